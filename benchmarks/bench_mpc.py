"""The preview MPC's cost: solve time, control tick, and a 600 s mission's CPU time against the robust FF.

    python -m benchmarks.bench_mpc [--duration 600] [--qps 2400]   # writes benchmarks/results/mpc.json

* **In-process, one process** (W3, seed 1): the control task's compute time per tick (the scheduler's
  own statistics: p50, p99), the MPC's solve time and iterations (its ``ctrl_ms``/``ctrl_iter``
  columns: everything the law does in a tick, the FF fallback it always computes included), and the
  mission's CPU time (``time.process_time``) for C-PD+FF and for the MPC; the aims are a tick p99 of at
  most 10 ms and a CPU ratio of at most 3.
* **The QP solvers on the same problems**: the QPs of a W3 mission are recorded and solved again by
  DAQP (the firmware's), and by OSQP and by CasADi's qpOASES when those are installed (they are not
  project dependencies: ``pip install osqp casadi`` to compare): failures, iterations, time, and the
  first move's distance from DAQP's exact solution in units of τ_max.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.common import write
from firmware_py.control import mpc_qp
from sitl.harness.results import COLUMN
from sitl.harness.run import run_mission
from sitl.harness.spec import RunSpec


def mission(controller: str, duration: float) -> dict:
    t0 = time.process_time()
    r = run_mission(RunSpec(case="W3", controller=controller, seed=1, duration=duration))
    cpu = time.process_time() - t0
    out = {"cpu_s": cpu, "wall_s": r.results["wall_time_s"], "control_tick_us": r.results["control_tick"],
           "rmse": r.results["rmse"]}
    if controller == "mpc":
        ms, it = r.timeseries[:, COLUMN["ctrl_ms"]], r.timeseries[:, COLUMN["ctrl_iter"]]
        out["solve_ms"] = {"p50": float(np.percentile(ms, 50)), "p99": float(np.percentile(ms, 99)),
                           "max": float(ms.max())}
        out["iterations"] = {"p50": float(np.percentile(it, 50)), "p99": float(np.percentile(it, 99)),
                             "max": float(it.max())}
        out["solver"] = r.results["solver"]
    return out


def record_qps(duration: float) -> list[tuple]:
    """The (P, q, A, lo, hi) of every tick's QP in a W3 mission (the MPC's own solver flies it)."""
    got: list[tuple] = []
    original = mpc_qp.daqp.solve

    def spy(P, q, A, hi, lo, **kw):
        got.append((np.array(P), np.array(q), np.array(A), np.array(lo), np.array(hi)))
        return original(P, q, A, hi, lo, **kw)
    mpc_qp.daqp.solve = spy
    try:
        run_mission(RunSpec(case="W3", controller="mpc", seed=2, duration=duration))
    finally:
        mpc_qp.daqp.solve = original
    return got


def compare_solvers(qps: list[tuple]) -> dict:
    """Each available solver on the recorded QPs, against DAQP's exact solutions."""
    import daqp

    exact, out = [], {}
    t, its = 0.0, []
    sense = None
    for P, q, A, lo, hi in qps:
        t0 = time.perf_counter()
        x, _, flag, info = daqp.solve(P, q, A, hi, lo, **({} if sense is None else {"sense": sense}))
        t += time.perf_counter() - t0
        lam = np.asarray(info["lam"])
        sense = np.where(lam > 0, 1, np.where(lam < 0, 3, 0)).astype(np.int32) if flag == 1 else None
        exact.append(np.asarray(x))
        its.append(info["iterations"])
    out["daqp_warm"] = {"failed": 0, "iterations_p50": float(np.median(its)), "iterations_p99":
                        float(np.percentile(its, 99)), "mean_ms": 1e3 * t / len(qps), "first_move_err_max": 0.0}
    try:
        import osqp
        import scipy.sparse as sp
    except ImportError:
        out["osqp"] = "not installed"
    else:
        for eps, iters in ((1e-3, 1000), (1e-4, 200), (1e-4, 1000)):
            m = osqp.OSQP()
            n = qps[0][0].shape[0]
            rows, cols = np.triu_indices(n)
            order = np.lexsort((rows, cols))
            rows, cols = rows[order], cols[order]
            m.setup(sp.csc_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n)), np.zeros(n),
                    sp.csc_matrix(qps[0][2]), -np.ones(qps[0][2].shape[0]), np.ones(qps[0][2].shape[0]),
                    verbose=False, warm_starting=True, polishing=False, adaptive_rho_interval=25, max_iter=iters,
                    eps_abs=eps, eps_rel=eps)
            bad, t, its, err = 0, 0.0, [], []
            for (P, q, _, lo, hi), x_exact in zip(qps, exact, strict=True):
                t0 = time.perf_counter()
                m.update(Px=P[rows, cols], q=q, l=lo, u=hi)
                r = m.solve(raise_error=False)
                t += time.perf_counter() - t0
                its.append(r.info.iter)
                if r.info.status_val not in (1, 2):
                    bad += 1
                else:
                    err.append(float(np.abs(r.x[:3] - x_exact[:3]).max()))
            out[f"osqp_eps{eps:g}_iter{iters}"] = {
                "failed": bad, "iterations_p50": float(np.median(its)), "iterations_p99": float(np.percentile(its, 99)),
                "mean_ms": 1e3 * t / len(qps), "first_move_err_p99": float(np.percentile(err, 99)) if err else None,
                "first_move_err_max": max(err) if err else None}
    try:
        import casadi as ca
    except ImportError:
        out["casadi_qpoases"] = "not installed"
    else:
        n, mrows = qps[0][0].shape[0], qps[0][2].shape[0]
        for name in ("qpoases", "daqp"):
            s = ca.conic("s", name, {"h": ca.Sparsity.dense(n, n), "a": ca.Sparsity.dense(mrows, n)},
                         {"error_on_fail": False, **({"printLevel": "none"} if name == "qpoases" else {})})
            bad, t = 0, 0.0
            for P, q, A, lo, hi in qps:
                t0 = time.perf_counter()
                s(h=P, g=q, a=A, lba=lo, uba=hi)
                t += time.perf_counter() - t0
                bad += int(not s.stats()["success"])
            out[f"casadi_{name}"] = {"failed": bad, "mean_ms": 1e3 * t / len(qps)}
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--qps", type=float, default=120.0, help="s of W3 whose QPs the solvers are compared on")
    args = ap.parse_args(argv)
    figures: dict = {"missions": {c: mission(c, args.duration) for c in ("cpd_ff", "mpc")}}
    m = figures["missions"]
    figures["cpu_ratio_mpc_to_ff"] = m["mpc"]["cpu_s"] / m["cpd_ff"]["cpu_s"]
    figures["aims"] = {"tick_p99_ms_at_most": 10.0, "cpu_ratio_at_most": 3.0}
    figures["solvers"] = compare_solvers(record_qps(args.qps))
    path = write("mpc", figures)
    for c, v in m.items():
        print(f"{c:7s} tick p50 {v['control_tick_us']['p50_us'] / 1e3:.2f} ms p99 "
              f"{v['control_tick_us']['p99_us'] / 1e3:.2f} ms, CPU {v['cpu_s']:.1f} s")
    print(f"CPU ratio MPC/FF {figures['cpu_ratio_mpc_to_ff']:.2f}; wrote {path}")
    return figures


if __name__ == "__main__":
    main()
