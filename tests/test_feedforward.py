"""The wave feed-forward laws (firmware_py/control/feedforward.py) against analytic truth and an extreme wave group.

Issue #11: the paper's law predicts the load on a vehicle *holding station*;
when a wave group carries the vehicle with the water it predicts a Munk
moment the vehicle does not feel, larger than the pitch authority, and tips
it. The robust law must not, in a focused 4.5 m crest over the station
(configs/sea/design/W2F.yaml, constrained NewWave), and must do no worse than C-PD.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from bridge.models.vehicle import BodyFlow, VehicleParams, restoring_forces, strip_nodes
from firmware_py.control.feedforward import WaveFeedForward
from firmware_py.params.table import load_params
from sitl.harness.run import build_mission, run_mission, take_off
from sitl.harness.spec import RunSpec
from sitl.sea import Sea

VEHICLE = VehicleParams.load("bluerov2_heavy")


def uniform_flow(u_p: float, w_p: float, ax: float = 0.0, az: float = 0.0) -> BodyFlow:
    """The same body-frame flow at every strip and all three stage instants."""
    xs, wts = strip_nodes(VEHICLE.length, 3)
    full = lambda v: np.full((3, xs.size), v)  # noqa: E731
    return BodyFlow(xs, wts, full(u_p), full(w_p), full(ax), full(az))


def ff_law(mode: int, **overrides) -> WaveFeedForward:
    return WaveFeedForward(VEHICLE, load_params(overrides={"WK_FF_MODE": mode, "WK_FF_VEL_TC": 0.0,
                                                           "WK_FF_MON_THR": 0.0, **overrides}))


# ----------------------------------------------------------------------------- the laws, analytically

def test_paper_law_predicts_the_munk_moment_of_the_whole_flow():
    """Vehicle at rest in a uniform flow (u_p, w_p): drag per axis and the Munk moment (Z_ẇ − X_u̇) u_p w_p."""
    u_p, w_p = 1.0, -0.8
    out = ff_law(0).update(uniform_flow(u_p, w_p), np.zeros(6))
    p = VEHICLE
    want = np.array([(p.X_u + p.X_uu * abs(u_p)) * u_p, (p.Z_w + p.Z_ww * abs(w_p)) * w_p,
                     (p.Z_wdot - p.X_udot) * u_p * w_p])
    np.testing.assert_allclose(out.tau_e_hat, want, rtol=1e-12)
    np.testing.assert_allclose(out.tau_ff, -want, rtol=1e-12)
    assert abs(want[2]) > 9.0      # ≈ 10 N m: more than half the 16.8 N m pitch authority


def test_robust_law_is_the_paper_law_for_a_vehicle_at_rest():
    flow = uniform_flow(0.4, 0.3, ax=0.2, az=-0.5)
    paper = ff_law(0).update(flow, np.zeros(6))
    robust = ff_law(1, WK_FF_LIM_X=2.0, WK_FF_LIM_Z=2.0, WK_FF_LIM_P=2.0).update(flow, np.zeros(6))
    np.testing.assert_allclose(robust.tau_e_hat, paper.tau_e_hat, rtol=1e-12, atol=1e-12)


def test_robust_law_sees_no_moment_on_a_vehicle_carried_by_the_water():
    """Moving with a uniform flow, the body feels no relative flow: no Munk moment, no strip moment.
    In surge and heave the load is the still-water damping the flow takes away, D(ν_p) ν_p."""
    u_p, w_p = 1.0, -0.8
    x_hat = np.array([0.0, 5.0, 0.0, u_p, w_p, 0.0])
    out = ff_law(1, WK_FF_LIM_X=2.0, WK_FF_LIM_Z=2.0, WK_FF_LIM_P=2.0).update(uniform_flow(u_p, w_p), x_hat)
    p = VEHICLE
    want = [(p.X_u + p.X_uu * abs(u_p)) * u_p, (p.Z_w + p.Z_ww * abs(w_p)) * w_p, 0.0]
    np.testing.assert_allclose(out.tau_e_hat, want, rtol=1e-12, atol=1e-12)
    # The wave part at the estimated velocity (mode 2) keeps a moment: minus the vehicle's own Munk moment
    wave_part = ff_law(2).update(uniform_flow(u_p, w_p), x_hat)
    assert wave_part.tau_e_hat[2] == pytest.approx(-(p.Z_wdot - p.X_udot) * u_p * w_p, rel=1e-12)


def test_robust_law_bounds_the_velocity_between_holding_station_and_the_water():
    """An estimate faster than the water counts as moving with it; one against the water as holding station."""
    u_p, w_p = 0.5, -0.3
    law = lambda: ff_law(1, WK_FF_LIM_X=2.0, WK_FF_LIM_Z=2.0, WK_FF_LIM_P=2.0)  # noqa: E731
    flow = uniform_flow(u_p, w_p)
    too_fast = law().update(flow, np.array([0.0, 5.0, 0.0, 2.0, -1.0, 0.0])).tau_e_hat
    with_water = law().update(flow, np.array([0.0, 5.0, 0.0, u_p, w_p, 0.0])).tau_e_hat
    np.testing.assert_allclose(too_fast, with_water, rtol=1e-12, atol=1e-12)
    against = law().update(flow, np.array([0.0, 5.0, 0.0, -1.0, 1.0, 0.0])).tau_e_hat
    np.testing.assert_allclose(against, ff_law(0).update(flow, np.zeros(6)).tau_e_hat, rtol=1e-12)


def test_robust_law_limits_its_authority_per_axis():
    """A flow whose load exceeds WK_FF_LIM_*·τ_max is clipped there; the prediction itself is not."""
    law = ff_law(1, WK_FF_LIM_X=0.5, WK_FF_LIM_Z=0.25, WK_FF_LIM_P=0.1)
    out = law.update(uniform_flow(-2.0, 2.0, ax=-3.0, az=3.0), np.zeros(6))
    tau_max = np.array(law.params.axes("WK_TAU_MAX"))
    np.testing.assert_allclose(np.abs(out.tau_ff), [0.5, 0.25, 0.1] * tau_max, rtol=1e-12)
    assert np.all(np.abs(out.tau_e_hat) > [0.5, 0.25, 0.1] * tau_max)
    assert np.all(np.sign(out.tau_ff) == -np.sign(out.tau_e_hat))


def test_monitor_fades_an_axis_whose_prediction_the_motion_contradicts():
    """The observer: a vehicle at rest, thrusters holding its 2 N of buoyancy, sees no load; a forecast
    predicting a large one fades, within a second, and recovers when the forecast agrees again."""
    law = WaveFeedForward(VEHICLE, load_params(overrides={"WK_FF_MODE": 1, "WK_FF_MON_THR": 0.1,
                                                         "WK_FF_MON_TC": 0.5}), 0.05)
    x_hat = np.array([0.0, 5.0, 0.0, 0.0, 0.0, 0.0])
    hover = restoring_forces(VEHICLE, x_hat[:3])                # τ = g(η): the thrust that holds it still
    assert hover[1] == pytest.approx(VEHICLE.B - VEHICLE.W)    # 2 N down against the net buoyancy
    wrong = uniform_flow(0.0, 0.0, ax=0.0, az=2.0)             # Z_ẇ·2 ≈ 37 N predicted, none observed
    for _ in range(20):
        out = law.update(wrong, x_hat, hover)
    assert out.weight[1] < 0.05 and out.weight[0] == pytest.approx(1.0) and abs(out.tau_ff[1]) < 2.0
    still = uniform_flow(0.0, 0.0)
    for _ in range(100):
        out = law.update(still, x_hat, hover)
    assert np.all(out.weight > 0.95)


# ----------------------------------------------------------------------------- the extreme wave group

@pytest.fixture(scope="module")
def focused_runs():
    """W2 with a 4.5 m crest over the station at t = 60 s: C-PD, paper FF, robust FF with and
    without the saturation preview (90 s each)."""
    sea = Sea.load("design/W2F")
    assert float(sea.elevation(0.0, 60.0)) == pytest.approx(4.5, abs=1e-9)
    spec = dict(case="design/W2F", duration=90.0)
    return {"cpd": run_mission(RunSpec(controller="cpd", **spec)).results,
            "paper": run_mission(RunSpec(controller="cpd_ff", overrides={"WK_FF_MODE": 0}, **spec)).results,
            "robust": run_mission(RunSpec(controller="cpd_ff", **spec)).results,
            "no_preview": run_mission(RunSpec(controller="cpd_ff", overrides={"WK_PRV_ENABLE": 0}, **spec)).results}


def test_robust_ff_rides_out_the_focused_crest_no_worse_than_cpd(focused_runs):
    cpd, ff = focused_runs["cpd"]["max_abs_error"], focused_runs["robust"]["max_abs_error"]
    assert math.degrees(ff["pitch"]) < 20.0
    assert ff["pitch"] <= cpd["pitch"] + math.radians(2.0)
    assert ff["surge"] <= cpd["surge"] + 0.1 and ff["heave"] <= cpd["heave"] + 0.1
    assert focused_runs["robust"]["ff_active_fraction"] > 0.95


def test_paper_ff_tips_the_vehicle_in_the_focused_crest(focused_runs):
    """The failure of issue #11, reproduced: so the test above can fail."""
    assert math.degrees(focused_runs["paper"]["max_abs_error"]["pitch"]) > 20.0
    assert math.degrees(focused_runs["cpd"]["max_abs_error"]["pitch"]) < 20.0


def test_saturation_preview_shrinks_the_excursion_the_thrusters_cannot_prevent(focused_runs):
    """The group's loads exceed τ_max in surge and heave: pre-positioning ahead of it leaves less to give."""
    with_, without = focused_runs["robust"]["max_abs_error"], focused_runs["no_preview"]["max_abs_error"]
    assert with_["heave"] < without["heave"] - 0.2
    assert with_["surge"] < without["surge"]


def test_monitor_announces_a_fade_and_logs_its_weight():
    """A useless forecast (−10 dB): the monitor fades FF, says so by STATUSTEXT, and the weights are logged."""
    m = build_mission(RunSpec("W2", "cpd_ff", -10.0, duration=40.0), params=load_params())
    fw = m.firmware
    take_off(m)
    weights = []
    for _ in range(600):
        fw.scheduler.run_tick()
        m.hal.step_world()
        weights.append(fw.last.ff_weight)
    assert min(w.min() for w in weights) < 0.5
    assert any(text.startswith("FF faded") for _, text in fw.events)
