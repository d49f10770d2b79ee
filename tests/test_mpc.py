"""The preview MPC (firmware_py/control/mpc.py) flying the simulated vehicle, with the real QP solver.

Against the laws it must beat or match (C-PD in still water, the robust FF under a known periodic
load), against the thrusters' limits it must never exceed, and against the firmware's discipline: a
solve out of budget flies the FF command that tick, no forecast is no crash, same seed same result.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from bridge.forecast import oracle_forecast
from bridge.models.horizon import horizon_grid, lag_profile, linearise_horizon
from bridge.models.thrusters import T200Curve, ThrusterLayout
from bridge.models.vehicle import VehicleParams
from bridge.models.waves import WaveComponents
from bridge.schemas import load_vehicle_config
from firmware_py.control.cascaded_pd import SolveStatus
from firmware_py.control.mpc_qp import block_expansion, prediction_matrix
from firmware_py.control.wrench_limits import WrenchPolytope
from sitl.harness.results import COLUMN
from sitl.harness.run import build_mission, run_mission, take_off
from sitl.harness.spec import RunSpec
from sitl.sea import Sea

LAYOUT = ThrusterLayout.from_config(load_vehicle_config("bluerov2_heavy")["thrusters"])
F_MAX = 35.0


def regular_sea(amplitude: float = 0.5, period: float = 8.0) -> Sea:
    """One linear wave: a known periodic load at the station."""
    w = 2 * math.pi / period
    comps = WaveComponents.from_spectrum_lines(np.array([amplitude]), np.array([w]), np.array([0.3]), 54.0, False)
    return Sea("regular", comps, lambda x: np.zeros_like(x), w, 4 * amplitude / math.sqrt(2), 0)


def fly(spec: RunSpec, seconds: float, sea: Sea | None = None, initial_eta=None, watch=None, prepare=None):
    """Fly the in-process mission tick by tick; ``prepare(mission)`` before take-off, ``watch(firmware)``
    after every tick."""
    m = build_mission(spec, initial_eta=initial_eta, sea=sea)
    if prepare is not None:
        prepare(m)
    take_off(m)
    for _ in range(int(round(seconds * m.rate_hz)) - 1):
        m.firmware.scheduler.run_tick()
        m.hal.step_world()
        if watch is not None:
            watch(m.firmware)
    return m


CURVE = T200Curve.from_config(load_vehicle_config("bluerov2_heavy")["thrusters"])


def solved_within_thrust_limits(run) -> None:
    """Every tick the law solved, and every thruster's commanded thrust (its logged PWM through the T200 curve)
    within ±WK_THR_MAX (whole-µs PWM: 0.2 N)."""
    log = run.timeseries
    assert (log[:, COLUMN["ctrl_status"]] == SolveStatus.SOLVED).all()
    pwm = log[:, [COLUMN[f"pwm{i}"] for i in range(1, 9)]]
    assert np.abs(CURVE.thrust(pwm.ravel())).max() <= F_MAX + 0.2


# ----------------------------------------------------------------------------- the limits

def test_the_blurov2_heavys_wrench_limits_are_its_thruster_pairs():
    """|X| ≤ 4 f cos 45°, |Z ± M / l_x| ≤ 4 f with l_x = 0.12 m (the vertical pairs), from the layout alone."""
    poly = WrenchPolytope.from_allocation(LAYOUT.allocation_matrix(), -F_MAX, F_MAX)
    assert poly.normals.shape == (3, 3)
    for tau, inside in (([4 * F_MAX * math.cos(math.pi / 4) - 1e-6, 0, 0], True), ([100.0, 0, 0], False),
                        ([140.0 - 1e-6, 0, 0], False), ([0, 139.999, 0], True), ([0, 100.0, 0.12 * 40.0], True),
                        ([0, 100.0, 0.12 * 40.1], False), ([0, 0, 16.79], True), ([0, 0, 16.81], False)):
        assert poly.contains(tau) == inside, tau
    # every wrench of the polytope is reached by the mixer's pseudo-inverse within the thrusters' limits
    rng = np.random.default_rng(0)
    pinv = np.linalg.pinv(LAYOUT.allocation_matrix())
    for f in rng.uniform(-F_MAX, F_MAX, size=(200, 8)):
        tau = LAYOUT.allocation_matrix() @ f
        assert poly.contains(tau)
        assert np.abs(pinv @ tau).max() <= F_MAX + 1e-9


# ----------------------------------------------------------------------------- the model

def test_the_horizon_rollout_is_uniform_acceleration_for_a_trimmed_undamped_body():
    """W = B, no damping, level, a held heave force F from rest: z = ½ F t²/(m + Z_ẇ) exactly (RK4 is exact on
    polynomials), and the Jacobian of the last state on the held demand is the same closed form."""
    p = VehicleParams.load("bluerov2_heavy")
    from dataclasses import replace
    p = replace(p, B=p.W, r_B=np.zeros(3), X_u=0, Z_w=0, M_q=0, X_uu=0, Z_ww=0, M_qq=0, X_udot=0.0, X_qdot=0.0)
    n, F = 10, 20.0
    dt = horizon_grid(0.05, 0.1, n)
    a_mid, _ = lag_profile(dt, 0.1)
    V = np.tile([0.0, F, 0.0], (n, 1))
    X, A, B, E = linearise_horizon(p, np.array([0.0, 5.0, 0.0, 0, 0, 0]), np.array([0.0, F, 0.0]), V, dt, a_mid,
                                   np.zeros(3), None)
    T = dt.sum()
    m = p.mass + p.Z_wdot
    assert X[-1, 1] - 5.0 == pytest.approx(0.5 * F / m * T**2, rel=1e-9)
    assert X[-1, 4] == pytest.approx(F / m * T, rel=1e-9)
    S = prediction_matrix(A, B, E)
    # a unit change of every demand (and so of the thrust after the first step) moves z_N by about T²/(2m)
    dz = S[-6 + 1] @ (block_expansion(n, 1) @ np.tile([0, 1.0, 0], n))
    assert dz == pytest.approx(0.5 * T**2 / m, rel=0.05)


# ----------------------------------------------------------------------------- the law in flight

@pytest.mark.parametrize("start", [[0.5, 4.5, 0.1], [3.0, 2.5, 0.0]])
def test_in_still_water_a_setpoint_step_is_held_as_well_as_cpd_and_within_the_thrusters_limits(start):
    """A step within the plan's error bound (WK_MPC_EMAX 2 m) and one beyond it (3 m in surge, 2.5 m in heave:
    corrected at a bounded pace, as C-PD's velocity limit bounds its own)."""
    step = dict(initial_eta=start, sea=Sea.still_water())
    cpd = run_mission(RunSpec(controller="cpd", duration=20.0), **step).results
    run = run_mission(RunSpec(controller="mpc", duration=20.0), **step)
    solved_within_thrust_limits(run)
    for dof in ("surge", "heave", "pitch"):
        assert run.results["rmse"][dof] <= cpd["rmse"][dof], dof
    assert run.results["solver"]["fallbacks"] == {"timeout": 0, "infeasible": 0, "nonfinite": 0, "failed": 0}


def test_a_known_periodic_load_with_its_exact_forecast_is_cancelled_at_least_as_well_as_ff():
    sea = regular_sea()
    ff = run_mission(RunSpec(controller="cpd_ff", duration=30.0), sea=sea).results
    run = run_mission(RunSpec(controller="mpc", duration=30.0), sea=sea)
    solved_within_thrust_limits(run)
    for dof in ("surge", "heave", "pitch"):
        assert run.results["rmse"][dof] <= ff["rmse"][dof], (dof, run.results["rmse"][dof], ff["rmse"][dof])


def on_the_wall_clock(m) -> None:
    """The law as it runs on a vehicle's wall clock, where the millisecond budget applies."""
    m.firmware.controller.wall_clock = True


def test_a_budget_the_solver_cannot_meet_flies_the_ff_command_every_tick():
    """A 10 µs budget on the wall clock: every solve is out of budget, so every tick flies the C-PD+FF command —
    the mission is the C-PD+FF mission to the bit — and the episode is announced once, not every tick."""
    spec = dict(case="W1", seed=3, duration=4.0)
    trace = {"ff": [], "mpc": []}
    texts: list[str] = []

    def watch(name):
        def see(fw):
            trace[name].append((fw.last.control.tau.copy(), fw.last.mix.pwm.copy(), fw.last.x_hat.copy()))
            if name == "mpc":
                assert fw.last.solve.status == SolveStatus.TIMEOUT
                texts.extend(t for _, t in fw.events if t.startswith("MPC"))
                fw.events.clear()
        return see
    fly(RunSpec(controller="cpd_ff", **spec), 4.0, watch=watch("ff"))
    fly(RunSpec(controller="mpc", overrides={"WK_MPC_BUDGET": 0.01}, **spec), 4.0, watch=watch("mpc"),
        prepare=on_the_wall_clock)
    assert len(trace["mpc"]) == len(trace["ff"]) > 70
    for (tau_f, pwm_f, x_f), (tau_m, pwm_m, x_m) in zip(trace["ff"], trace["mpc"], strict=True):
        np.testing.assert_array_equal(tau_m, tau_f)
        np.testing.assert_array_equal(pwm_m, pwm_f)
        np.testing.assert_array_equal(x_m, x_f)
    assert texts == ["MPC: flying FF, out of budget"]


def test_in_lockstep_the_budget_is_the_solvers_iteration_limit():
    """In lockstep SITL the budget is counted in iterations (a run is the same on any machine): one iteration
    is too few where the thrusters' limits bind, so those ticks time out, are counted, and fly the FF."""
    r = run_mission(RunSpec(controller="mpc", case="W3", seed=2, duration=6.0, overrides={"WK_MPC_ITER": 1}))
    status = r.timeseries[:, COLUMN["ctrl_status"]]
    assert (status == SolveStatus.TIMEOUT).mean() > 0.5
    assert set(np.unique(status)) <= {SolveStatus.SOLVED, SolveStatus.TIMEOUT}
    summary = r.results["solver"]
    assert summary["fallbacks"]["timeout"] == int((status == SolveStatus.TIMEOUT).sum())
    assert summary["iterations"]["max"] <= 1


def test_no_forecast_is_mpc_on_the_vehicle_model_alone():
    """A forecast that expires mid-flight: the MPC goes on solving, in still water, and the vehicle is held."""
    m = build_mission(RunSpec(controller="mpc", case="W1", duration=5.0))
    short = oracle_forecast(m.sea.components, None, None, valid_until=2.0)
    m.firmware.forecast.offer(short)
    take_off(m)
    for _ in range(99):
        m.firmware.scheduler.run_tick()
        m.hal.step_world()
        assert m.firmware.last.solve.status == SolveStatus.SOLVED
        assert np.isfinite(m.firmware.last.control.tau).all()
    assert not m.firmware.last.ff_active
    assert abs(m.plant.state.eta[1] - 5.0) < 0.5


def test_the_same_seed_gives_the_same_mission():
    spec = RunSpec(controller="mpc", case="W3", seed=7, duration=3.0)
    a, b = run_mission(spec), run_mission(spec)
    cols = [i for name, i in COLUMN.items() if name != "ctrl_ms"]
    np.testing.assert_array_equal(a.timeseries[:, cols], b.timeseries[:, cols])
    assert a.results["rmse"] == b.results["rmse"]
