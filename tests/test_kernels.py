"""The compiled kernels (bridge/models/kernels.py) against the numpy/Python reference path.

Each public entry point is called twice on the same inputs: with the kernels
(the default when numba is installed) and with ``kernels.ENABLED`` off (the
reference, unchanged from before the kernels). They agree to 1e-12 relative to
the size of the quantity; a whole mission on the two paths agrees to 1e-9.

Agreement alone would pass a physics error made in both, so every kernel family
also meets a value worked out here by hand, on each path (the ``path`` fixture):
the Stokes kinematics at the strips, the still-water load, the rates of a cruising
and of a released vehicle, an RK4 heave decay, the Jacobian's linearisation, the
preview's coast, the pseudo-inverse allocation and the T200's published samples.
The wave-load checks hold in still water, whatever the model adds for the waves.
"""
from __future__ import annotations

import numpy as np
import pytest

from bridge.models import kernels
from bridge.models.vehicle import (
    VehicleParams,
    body_flow,
    hydrodynamic_load_at,
    rates_jacobian,
    rk4_step,
    state_rates_at,
    strip_nodes,
    wave_load,
)
from sitl.sea import Sea

needs_numba = pytest.mark.skipif(not kernels.ENABLED, reason="numba not installed or WAVEKEEP_NUMBA=0")


@pytest.fixture(scope="module")
def vehicle() -> VehicleParams:
    return VehicleParams.load("bluerov2_heavy")


@pytest.fixture(scope="module")
def sea() -> Sea:
    return Sea.load("W3")


@pytest.fixture(params=["compiled", "reference"])
def path(request, monkeypatch) -> str:
    """Run the test on the compiled kernels, then on the reference path."""
    if request.param == "compiled" and not kernels.ENABLED:
        pytest.skip("numba not installed or WAVEKEEP_NUMBA=0")
    monkeypatch.setattr(kernels, "ENABLED", request.param == "compiled")
    return request.param


def both(monkeypatch, fn):
    """fn() with the kernels, then with the reference path."""
    fast = fn()
    monkeypatch.setattr(kernels, "ENABLED", False)
    ref = fn()
    monkeypatch.setattr(kernels, "ENABLED", True)
    return fast, ref


def close(a, b, scale=None, tol=1e-12):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = float(np.max(np.abs(b))) if scale is None else scale
    assert np.max(np.abs(a - b)) <= tol * max(scale, 1e-300), (a, b)


@needs_numba
@pytest.mark.parametrize("strips", [1, 3, 6])
@pytest.mark.parametrize("pose", [(0.0, 5.0, 0.0), (3.2, 1.1, 0.3), (-7.0, 0.05, -0.4), (1.0, 80.0, 0.1)])
def test_body_flow_matches_numpy(monkeypatch, sea, vehicle, strips, pose):
    xs = strip_nodes(vehicle.length, strips)
    t = 123.4 + np.array([0.0, 0.025, 0.05])
    fast, ref = both(monkeypatch, lambda: body_flow(sea.components, np.array(pose), t, xs))
    for name in ("u", "w", "ax", "az"):
        close(getattr(fast, name), getattr(ref, name))


@needs_numba
def test_body_flow_linear_sea_and_one_time(monkeypatch, sea, vehicle):
    from dataclasses import replace
    linear = replace(sea.components, second_order=False)
    xs = strip_nodes(vehicle.length, 3)
    fast, ref = both(monkeypatch, lambda: body_flow(linear, np.array([0.5, 4.0, 0.05]), 17.0, xs))
    assert fast.u.shape == ref.u.shape == (1, 3)
    for name in ("u", "w", "ax", "az"):
        close(getattr(fast, name), getattr(ref, name))


@needs_numba
def test_loads_rates_rk4_and_jacobian_match_python(monkeypatch, sea, vehicle):
    rng = np.random.default_rng(4)
    xs = strip_nodes(vehicle.length, 3)
    for _ in range(20):
        x = np.array([rng.normal(), rng.uniform(0.0, 8.0), rng.normal(0, 0.3), *rng.normal(0, 0.5, 3)])
        tau = rng.normal(0, 40.0, (3, 3))
        flow = body_flow(sea.components, x[:3], rng.uniform(0, 600) + np.array([0.0, 0.025, 0.05]), xs)
        for f in (flow, None):
            for i in range(3):
                fast, ref = both(monkeypatch, lambda f=f, i=i, x=x: hydrodynamic_load_at(vehicle, *x[3:], f, i))
                close(fast, ref)
                fast, ref = both(monkeypatch, lambda f=f, i=i, x=x, tau=tau: state_rates_at(vehicle, x, tau[i], f, i))
                close(fast, ref)
            fast, ref = both(monkeypatch, lambda f=f, x=x, tau=tau: rk4_step(vehicle, x, 0.05, tau, f))
            close(fast, ref)
            fast, ref = both(monkeypatch, lambda f=f, x=x, tau=tau: rates_jacobian(vehicle, x, tau[0], f, 0))
            close(fast, ref)


@needs_numba
def test_wave_load_matches_python(monkeypatch, sea, vehicle):
    xs = strip_nodes(vehicle.length, 3)
    t = np.linspace(0.0, 30.0, 7)
    fast, ref = both(monkeypatch, lambda: wave_load(vehicle, sea.components, [0.0, 5.0, 0.02], [0.1, -0.2, 0.05],
                                                    t, xs))
    close(fast, ref)


@needs_numba
def test_allocation_matches_python_bit_for_bit(monkeypatch):
    """The mixer's allocation kernel is its float reference's operations one for one: equal bits, non-finite
    and signed-zero demands included."""
    from bridge.models.thrusters import T200Curve, ThrusterLayout
    from bridge.schemas import load_vehicle_config
    from firmware_py.motors.mixer import MotorMixer
    from firmware_py.params.table import load_params

    cfg = load_vehicle_config("bluerov2_heavy")["thrusters"]
    mixer = MotorMixer(ThrusterLayout.from_config(cfg), T200Curve.from_config(cfg), load_params(), 0.05)
    rng = np.random.default_rng(17)
    for k in range(2000):
        tau = rng.normal(0.0, float(rng.choice([1.0, 100.0, 1e5])), 3)
        if k % 4 == 0:
            tau[rng.integers(3)] = rng.choice([0.0, -0.0, np.inf, -np.inf, np.nan, 1e308])
        f_max = float(rng.choice([35.0, 1.0, 60.0]))
        fast, ref = both(monkeypatch, lambda t=tau, m=f_max: mixer.allocate(t, m))
        assert np.array_equal(fast.view(np.int64), ref.view(np.int64)), tau


@needs_numba
def test_t200_command_matches_python_bit_for_bit(monkeypatch):
    """The T200 curve's whole-µs command, compiled, against its reference and the array path: equal PWM and bits
    at the tables' knots and their neighbouring floats, zero, NaN, ±inf and beyond the limits."""
    from bridge.models.thrusters import T200Curve
    from bridge.schemas import load_vehicle_config

    curve = T200Curve.from_config(load_vehicle_config("bluerov2_heavy")["thrusters"])
    rng = np.random.default_rng(19)
    tables = np.concatenate([curve._fwd_f, curve._rev_f])
    f = np.concatenate([rng.uniform(-45.0, 55.0, 40000), rng.uniform(-1e-3, 1e-3, 8000), tables,
                        np.nextafter(tables, 100.0), np.nextafter(tables, -100.0),
                        [0.0, -0.0, np.nan, np.inf, -np.inf, curve.thrust_min, curve.thrust_max, 5e-324]])
    for chunk in np.array_split(f, len(f) // 8):
        (pwm, thrust), (pwm_ref, thrust_ref) = both(monkeypatch, lambda c=chunk: curve.command(c.tolist()))
        assert pwm.dtype == pwm_ref.dtype == np.int64 and np.array_equal(pwm, pwm_ref), chunk
        assert np.array_equal(thrust.view(np.int64), thrust_ref.view(np.int64)), chunk
    pwm_array = np.rint(curve.pwm(f.reshape(1, -1))[0]).astype(np.int64)        # the array path, as mix() had it
    pwm, thrust = curve.command(f.tolist())
    assert np.array_equal(pwm, pwm_array)
    assert np.array_equal(thrust.view(np.int64), curve.thrust(pwm_array.reshape(1, -1))[0].view(np.int64))


@needs_numba
@pytest.mark.processes
def test_a_mission_on_both_paths_agrees_to_1e9(monkeypatch):
    """Summation order moves last bits (the kernels sum per component, numpy's BLAS in blocks); through a
    closed loop with whole-µs PWM that stays below 1e-9 relative in every result."""
    from sitl.harness.run import run_mission
    from sitl.harness.spec import RunSpec

    spec = RunSpec("W3", "cpd_ff", duration=20.0)
    fast, ref = both(monkeypatch, lambda: run_mission(spec).results)
    for key in ("rmse", "max_abs_error", "mean_power_w"):
        for dof, v in ref[key].items():
            assert fast[key][dof] == pytest.approx(v, rel=1e-9, abs=1e-15), (key, dof)


# ---------------------------------------------------------------------------- analytic values, on both paths

G = 9.81          # m/s², as the models take it
KGF = 9.80665     # N per kgf (standard gravity)


@pytest.fixture(scope="module")
def cfg() -> dict:
    """Table II and the layout as the config file gives them (the models' inputs, read here independently)."""
    from bridge.schemas import load_vehicle_config
    return load_vehicle_config("bluerov2_heavy")


def mass_matrix(cfg: dict) -> np.ndarray:
    """M = M_RB + M_A about the CG (planar, Fossen 2011 Eq. 3.44), from Table II."""
    mp, am = cfg["mass_properties"], cfg["added_mass"]
    m, (x_g, _, z_g) = mp["W"] / G, mp["r_G"]
    M_RB = np.array([[m, 0.0, m * z_g], [0.0, m, -m * x_g], [m * z_g, -m * x_g, mp["I_y"]]])
    M_A = np.array([[am["X_udot"], 0.0, am["X_qdot"]], [0.0, am["Z_wdot"], 0.0], [am["X_qdot"], 0.0, am["M_qdot"]]])
    return M_RB + M_A


def test_body_flow_is_the_stokes_kinematics_at_each_strip(path, vehicle):
    """Body flow: two components of a 2nd-order finite-depth sea (Dean & Dalrymple, with cosh and sinh written
    out; k from the dispersion relation solved here), at the strips of a pitched body, in its frame."""
    from scipy.optimize import brentq

    from bridge.models.waves import WaveComponents

    d = 54.0
    omega, amp, eps = np.array([0.55, 0.9]), np.array([1.2, 0.4]), np.array([0.3, -1.1])
    k = np.array([brentq(lambda k, w=w: G * k * np.tanh(k * d) - w * w, 1e-6, 10.0, xtol=1e-15) for w in omega])
    xs = strip_nodes(vehicle.length, 3)
    x0, z0, th = 3.0, 5.0, 0.2
    t = np.array([10.0, 10.05])
    flow = body_flow(WaveComponents(amp, omega, k, eps, d), np.array([x0, z0, th]), t, xs)
    e_x, e_z = np.array([np.cos(th), -np.sin(th)]), np.array([np.sin(th), np.cos(th)])   # body axes in (N, D)
    for i, ti in enumerate(t):
        for j, xp in enumerate(xs[0]):
            x, s = x0 + xp * np.cos(th), z0 - xp * np.sin(th)            # the strip's place, s its depth
            ph = k * x - omega * ti + eps
            ch1, sh1 = np.cosh(k * (d - s)) / np.sinh(k * d), np.sinh(k * (d - s)) / np.sinh(k * d)
            ch2, sh2 = np.cosh(2 * k * (d - s)) / np.sinh(k * d) ** 4, np.sinh(2 * k * (d - s)) / np.sinh(k * d) ** 4
            b = 0.75 * omega * k * amp ** 2
            u = np.sum(amp * omega * ch1 * np.cos(ph) + b * ch2 * np.cos(2 * ph))
            w_up = np.sum(amp * omega * sh1 * np.sin(ph) + b * sh2 * np.sin(2 * ph))
            du = np.sum(amp * omega ** 2 * ch1 * np.sin(ph) + 2 * omega * b * ch2 * np.sin(2 * ph))      # ∂u/∂t
            dw_up = -np.sum(amp * omega ** 2 * sh1 * np.cos(ph) + 2 * omega * b * sh2 * np.cos(2 * ph))
            v, a = np.array([u, -w_up]), np.array([du, -dw_up])          # NED: w positive down
            got = [flow.u[i, j], flow.w[i, j], flow.ax[i, j], flow.az[i, j]]
            want = [v @ e_x, v @ e_z, a @ e_x, a @ e_z]
            close(got, want, scale=float(np.max(np.abs(want))), tol=1e-11)


def test_still_water_load_is_damping_and_the_added_mass_coriolis_force(path, vehicle, cfg):
    """Hydro load, in still water: −D(ν)ν − C_A(ν)ν, with C_A(ν)ν from the 6-DoF added-mass momenta by cross
    products (Fossen 2011 Eq. 6.43: [ν₂ × p₁, ν₁ × p₁ + ν₂ × p₂]); for pure translation the Munk moment."""
    am, dp = cfg["added_mass"], cfg["damping"]
    M_A = np.zeros((6, 6))
    M_A[0, 0], M_A[2, 2], M_A[4, 4] = am["X_udot"], am["Z_wdot"], am["M_qdot"]
    M_A[0, 4] = M_A[4, 0] = am["X_qdot"]
    for u, w, q in [(0.6, 0.0, 0.0), (0.0, -0.4, 0.0), (0.0, 0.0, 0.5), (0.5, 0.3, 0.0), (-0.3, 0.2, -0.4)]:
        nu = np.array([u, 0.0, w, 0.0, q, 0.0])
        p = M_A @ nu
        force, moment = np.cross(nu[3:], p[:3]), np.cross(nu[:3], p[:3]) + np.cross(nu[3:], p[3:])
        damping = [(dp["X_u"] + dp["X_uu"] * abs(u)) * u, (dp["Z_w"] + dp["Z_ww"] * abs(w)) * w,
                   (dp["M_q"] + dp["M_qq"] * abs(q)) * q]
        want = -np.array([force[0], force[2], moment[1]]) - damping
        got = hydrodynamic_load_at(vehicle, u, w, q, None)
        close(got, want, scale=float(np.max(np.abs(want))))
        if q == 0.0:
            assert got[2] == pytest.approx((am["Z_wdot"] - am["X_udot"]) * u * w, rel=1e-12, abs=1e-15)


def test_rates_of_a_cruising_and_of_a_released_vehicle(path, vehicle, cfg):
    """State rates: the thrust that balances the damping at 0.8 m/s and the 2 N of net buoyancy holds a cruise
    (ν̇ = 0, η̇ = [u, 0, 0]); at rest, pitched and pushed, M ν̇ = τ − g(η) (Fossen 2011 Eq. 4.6)."""
    mp, dp = cfg["mass_properties"], cfg["damping"]
    W, B, u = mp["W"], mp["B"], 0.8
    cruise = state_rates_at(vehicle, np.array([0.0, 5.0, 0.0, u, 0.0, 0.0]),
                            np.array([(dp["X_u"] + dp["X_uu"] * u) * u, B - W, 0.0]))
    close(cruise, [u, 0.0, 0.0, 0.0, 0.0, 0.0], scale=1.0)
    th, tau = 0.1, np.array([20.0, -10.0, 1.5])
    BG_x = mp["r_G"][0] * W - mp["r_B"][0] * B
    BG_z = mp["r_G"][2] * W - mp["r_B"][2] * B
    g_eta = np.array([(W - B) * np.sin(th), -(W - B) * np.cos(th), BG_z * np.sin(th) + BG_x * np.cos(th)])
    released = state_rates_at(vehicle, np.array([1.0, 5.0, th, 0.0, 0.0, 0.0]), tau)
    close(released, [0.0, 0.0, 0.0, *np.linalg.solve(mass_matrix(cfg), tau - g_eta)])


def test_rk4_follows_the_closed_form_heave_decay(path, vehicle, cfg):
    """RK4: heave released at 0.5 m/s with the net buoyancy trimmed out, (m + Z_ẇ) ẇ = −(Z_w + Z_w|w| w) w:
    w(t) = a w₀ e^{−at/m'} / (a + b w₀ (1 − e^{−at/m'})), z(t) = z₀ + (m'/b) ln(1 + (b w₀/a)(1 − e^{−at/m'}));
    forty 50 ms steps end within RK4's error of it (1e-7 m/s, 3e-6 m: it falls 16-fold when h halves), where a
    wrong stage or weight, or a 2nd-order method, is off by 1e-4 to 1e-3."""
    mp, a, b = cfg["mass_properties"], cfg["damping"]["Z_w"], cfg["damping"]["Z_ww"]
    m_w = mp["W"] / G + cfg["added_mass"]["Z_wdot"]
    z0, w0, h, n = 5.0, 0.5, 0.05, 40
    tau = np.tile([0.0, mp["B"] - mp["W"], 0.0], (3, 1))
    x = np.array([0.0, z0, 0.0, 0.0, w0, 0.0])
    for _ in range(n):
        x = rk4_step(vehicle, x, h, tau)
    e = np.exp(-a * n * h / m_w)
    assert x[4] == pytest.approx(a * w0 * e / (a + b * w0 * (1.0 - e)), abs=1e-6)
    assert x[1] == pytest.approx(z0 + m_w / b * np.log(1.0 + b * w0 / a * (1.0 - e)), abs=1e-5)
    assert np.max(np.abs(x[[0, 2, 3, 5]])) < 1e-12                # surge and pitch stay still


def test_jacobian_is_the_hand_linearisation_of_a_cruise(path, vehicle, cfg):
    """Jacobian: ∂ẋ/∂x at u = 0.5 m/s, level, in still water, against its linearisation by hand: J(η) and its
    pitch derivative; −∂g/∂θ; the damping's 2X_u|u||u|; the Coriolis terms (m + X_u̇) u and the Munk (Z_ẇ − X_u̇) u."""
    mp, am, dp = cfg["mass_properties"], cfg["added_mass"], cfg["damping"]
    W, B, u, m = mp["W"], mp["B"], 0.5, mp["W"] / G
    A = rates_jacobian(vehicle, np.array([0.0, 5.0, 0.0, u, 0.0, 0.0]), np.zeros(3))
    want = np.zeros((6, 6))
    want[0, 3] = want[1, 4] = want[2, 5] = 1.0                    # J(0)
    want[1, 2] = -u                                               # ∂ż/∂θ = −u cos θ − w sin θ
    dr = np.zeros((3, 6))                                         # ∂(τ + F_h − C_RB ν − g)/∂x
    dr[:, 2] = [-(W - B), 0.0, -(mp["r_G"][2] * W - mp["r_B"][2] * B)]
    dr[0, 3] = -(dp["X_u"] + 2.0 * dp["X_uu"] * u)
    dr[1, 4], dr[1, 5] = -dp["Z_w"], (m + am["X_udot"]) * u
    dr[2, 4], dr[2, 5] = (am["Z_wdot"] - am["X_udot"]) * u, -dp["M_q"]
    want[3:] = np.linalg.solve(mass_matrix(cfg), dr)
    np.testing.assert_allclose(A, want, rtol=1e-5, atol=1e-4)     # forward differences, step 1e-6


def test_preview_coasts_as_its_euler_steps_say(path, vehicle, cfg):
    """Preview: with no gains and a calm sea, each axis coasts from ν₀ under linear damping; its explicit-Euler
    steps v_{j+1} = r v_j, r = 1 − Δt X_u/(m + X_u̇), give the excursion Δt v₀ r (1 − rⁿ)/(1 − r) in closed form."""
    from dataclasses import replace

    from bridge.models.waves import WaveComponents
    from firmware_py.control.preview import preview_excursions
    from firmware_py.params.table import load_params

    linear = replace(vehicle, X_uu=0.0, Z_ww=0.0)
    params = load_params()
    dt = params["WK_PRV_DT"]
    n = int(round(params["WK_PRV_HORIZON"] / dt))
    calm = WaveComponents(np.zeros(2), np.array([0.5, 0.8]), np.array([0.03, 0.07]), np.zeros(2), 54.0)
    gains = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [1.0, 1.0], [100.0, 100.0], [100.0, 100.0]])
    v0 = np.array([0.4, -0.3])
    cands = np.array([[-0.5, -0.5], [0.0, 0.0], [0.5, 0.5]])
    worst = preview_excursions(linear, params, calm, np.array([0.0, 5.0, 0.0]), np.array([*v0, 0.0]), np.zeros(2),
                               np.zeros(2), cands, 0.0, strip_nodes(vehicle.length, 3), gains)
    m = cfg["mass_properties"]["W"] / G
    r = 1.0 - dt * np.array([cfg["damping"]["X_u"] / (m + cfg["added_mass"]["X_udot"]),
                             cfg["damping"]["Z_w"] / (m + cfg["added_mass"]["Z_wdot"])])
    coast = np.abs(dt * v0 * r * (1.0 - r ** n) / (1.0 - r))
    close(worst, np.tile(coast, (3, 1)), tol=1e-12)


def test_allocation_is_the_layout_pseudo_inverse_and_saturates_pitch_first(path, cfg):
    """Allocation: B's rows are orthogonal (surge ∓cos 45° on the horizontals, heave 1 and pitch ∓l_x on the
    verticals), so B⁺τ shares each axis equally; beyond ±f_max pitch is served first and the rest gets the room
    left: four horizontals at 35 N give 140 cos 45° N of surge, four verticals 4 · 35 · l_x N m of pitch."""
    from bridge.models.thrusters import T200Curve, ThrusterLayout
    from firmware_py.motors.mixer import MotorMixer
    from firmware_py.params.table import load_params

    th = cfg["thrusters"]
    mixer = MotorMixer(ThrusterLayout.from_config(th), T200Curve.from_config(th), load_params(), 0.05)
    c, lx = np.sqrt(0.5), abs(th["layout"][4]["position"][0])
    X, Z, M = 20.0, -30.0, 2.0
    front, rear = Z / 4 - M / (4 * lx), Z / 4 + M / (4 * lx)
    close(mixer.allocate(np.array([X, Z, M]), 35.0),
          [-X / (4 * c), -X / (4 * c), X / (4 * c), X / (4 * c), front, front, rear, rear], tol=1e-8)
    close(mixer.allocate(np.array([300.0, 0.0, 0.0]), 35.0), [-35.0, -35.0, 35.0, 35.0, 0, 0, 0, 0], scale=35.0)
    f = mixer.allocate(np.array([0.0, 200.0, 20.0]), 35.0)        # pitch alone needs 20 / (4 l_x) = 41.7 N
    close(f, [0, 0, 0, 0, -35.0, -35.0, 35.0, 35.0], scale=35.0)
    close(mixer.B @ f, [0.0, 0.0, 4 * 35.0 * lx], scale=35.0)


def test_t200_command_gives_the_published_samples(path, cfg):
    """T200 command: each published thrust (kgf · 9.80665), and one a hair either side of it, is commanded at the
    sample's PWM, the nearest whole µs, and gives the published thrust; zero is the 1500 µs stop; beyond the
    limits the command saturates at 1100 / 1900 µs."""
    from bridge.models.thrusters import T200Curve

    curve = T200Curve.from_config(cfg["thrusters"])
    pwm_us, kgf = cfg["thrusters"]["curve"]["pwm_us"], cfg["thrusters"]["curve"]["thrust_kgf"]
    samples = [(p, f * KGF) for p, f in zip(pwm_us, kgf, strict=True) if f != 0.0]
    for hair in (0.0, 1e-9, -1e-9):
        pwm, thrust = curve.command([f * (1.0 + hair) for _, f in samples] + [0.0, 500.0, -500.0])
        assert pwm.tolist() == [p for p, _ in samples] + [1500, 1900, 1100], hair
        close(thrust, [f for _, f in samples] + [0.0, 5.25 * KGF, -4.07 * KGF], scale=5.25 * KGF)


@needs_numba
def test_the_horizon_rollout_and_its_jacobians_match_python(monkeypatch, sea, vehicle):
    """The MPC's horizon (bridge/models/horizon.py) on both paths: the rollout to 1e-12; the compiled path's exact
    Jacobians against the reference's forward differences to 1e-5 of their scale (the differences' truncation,
    ½·1e-6·|f''| with the quadratic drag's f'' ≈ 2 X_u|u|/(m + X_u̇) per (m/s)², reaches 1e-6)."""
    from bridge.models.horizon import horizon_grid, lag_profile, linearise_horizon, stage_times
    from firmware_py.control.mpc_qp import prediction_matrix

    dt = horizon_grid(0.05, 0.1, 12)
    a_mid, _ = lag_profile(dt, 0.1)
    offsets, a, b = stage_times(dt)
    x0 = np.array([0.2, 5.1, 0.03, 0.1, -0.2, 0.05])
    f = body_flow(sea.components, x0[:3], 40.0 + offsets, strip_nodes(vehicle.length, 3))
    flow = type(f)(f.xs, f.wts, 0.5 * (f.u[a] + f.u[b]), 0.5 * (f.w[a] + f.w[b]), 0.5 * (f.ax[a] + f.ax[b]),
                   0.5 * (f.az[a] + f.az[b]))
    V = np.random.default_rng(4).normal(0.0, 20.0, size=(12, 3))
    args = (vehicle, x0, np.array([5.0, -10.0, 1.0]), V, dt, a_mid, np.array([1.0, 2.0, 0.1]))
    for fl in (flow, None):
        fast, ref = both(monkeypatch, lambda fl=fl: linearise_horizon(*args, fl))
        close(fast[0], ref[0])
        for got, want in zip(fast[1:], ref[1:], strict=True):
            close(got, want, tol=1e-5)
        S_fast, S_ref = both(monkeypatch, lambda r=ref: prediction_matrix(*r[1:]))
        close(S_fast, S_ref)


def test_the_prediction_matrix_is_the_stacked_recursion(path):
    """δx_{k+1} = A δx_k + B δv_k + E δv_{k−1} with fixed A, B, E: block (k, j) of S is A^{k−j} B + A^{k−j−1} E
    (and B on the diagonal), written out by matrix powers."""
    from firmware_py.control.mpc_qp import prediction_matrix

    rng = np.random.default_rng(2)
    A, B, E = 0.3 * rng.normal(size=(6, 6)), rng.normal(size=(6, 3)), rng.normal(size=(6, 3))
    n = 5
    S = prediction_matrix(np.tile(A, (n, 1, 1)), np.tile(B, (n, 1, 1)), np.tile(E, (n, 1, 1)))
    power = [np.linalg.matrix_power(A, i) for i in range(n)]
    for k in range(n):
        for j in range(n):
            want = np.zeros((6, 3)) if j > k else power[k - j] @ B + (power[k - j - 1] @ E if k > j else 0.0)
            close(S[6 * k:6 * k + 6, 3 * j:3 * j + 3], want, scale=1.0)


@needs_numba
@pytest.mark.parametrize("x", [[0.2, 5.1, 0.03, 0.1, -0.2, 0.05], [-1.0, 0.08, -0.3, 0.6, 0.4, -0.7],
                               [0.0, 5.0, 0.0, -0.01, 0.02, 0.003]])
def test_the_analytic_jacobians_are_the_central_differences_of_the_rates_and_the_rk4_step(sea, vehicle, x):
    """The MPC horizon's exact linearisation (bridge/models/horizon_kernels.py) against central differences
    (step 1e-6, truncation ≈ 1e-12 of the scale away from a zero relative velocity, where v|v| has no second
    derivative): ∂f/∂x of the rates in still water and in the flow (a pose near the surface, where the
    buoyancy fades with z, included), and the RK4 step's ∂F/∂x, ∂F/∂v, ∂F/∂v_prev."""

    pv, x = vehicle.kernel_params, np.array(x)
    f = body_flow(sea.components, x[:3], 40.0 + np.array([0.0, 0.05, 0.1]), strip_nodes(vehicle.length, 3))
    z3 = np.zeros((3, 1))
    tau = np.array([[5.0, -10.0, 1.0], [6.0, -8.0, 0.5], [7.0, -6.0, 0.0]])
    sig_v, sig_p = np.array([0.0, 0.4, 0.4, 1.0]), np.array([1.0, 0.6, 0.6, 0.0])
    for flow in ((False, np.zeros(1), np.ones(1), z3, z3, z3, z3), (True, f.xs, f.wts, f.u, f.w, f.ax, f.az)):
        _check_linearisation(pv, x, tau, sig_v, sig_p, flow)


def _central(fn, x: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """∂fn/∂x by central differences, one column per component of x."""
    return np.stack([(fn(x + eps * e) - fn(x - eps * e)) / (2 * eps) for e in np.eye(x.size)], axis=1)


def _check_linearisation(pv, x, tau, sig_v, sig_p, flow) -> None:
    from bridge.models import horizon_kernels as hk

    has, xs, wts, up, wp, ax, az = flow
    J = hk.rates_jacobian_arr(pv, x, has, xs, wts, up[0], wp[0])
    close(J, _central(lambda y: kernels.state_rates_arr(pv, y, tau[0], has, xs, wts, up[0], wp[0], ax[0], az[0]), x),
          tol=1e-8)

    def step(y, dv, dp):
        st = tau + np.outer(sig_v[[0, 1, 3]], dv) + np.outer(sig_p[[0, 1, 3]], dp)
        return kernels.rk4_arr(pv, y, 0.1, st, has, xs, wts, up, wp, ax, az)
    z = np.zeros(3)
    xn, F, Bv, Ep = hk.rk4_linearised_arr(pv, x, 0.1, tau, sig_v, sig_p, has, xs, wts, up, wp, ax, az)
    close(xn, step(x, z, z), tol=0.0)          # the rollout: rk4_arr's bits
    close(F, _central(lambda y: step(y, z, z), x), tol=1e-8)
    close(Bv, _central(lambda v: step(x, v, z), z), tol=1e-8)
    close(Ep, _central(lambda v: step(x, z, v), z), tol=1e-8)


@needs_numba
def test_the_horizon_flow_by_angle_addition_is_the_flow_at_those_times(sea, vehicle):
    """The MPC's flow along its horizon (time phases from cos/sin(ω o_i) built once per forecast, shifted to each
    tick's start by angle addition) against body_flow at the instants t0 + o_i, late in a mission (t0 = 3000 s,
    where ω t is largest): equal to 1e-12 of the flow's scale, velocities and accelerations."""
    from bridge.models.horizon import OffsetPhases, horizon_flow, horizon_grid, stage_times

    offsets, _, _ = stage_times(horizon_grid(0.05, 0.1, 40), exact_steps=1)
    phases = OffsetPhases(sea.components, offsets)
    strips = strip_nodes(vehicle.length, 6)
    for t0, pose in ((12.35, (0.1, 5.0, 0.02)), (3000.05, (-0.4, 4.7, -0.1))):
        got = horizon_flow(phases, np.array(pose), t0, strips)
        want = body_flow(sea.components, np.array(pose), t0 + offsets, strips)
        for a, b in zip((got.u, got.w, got.ax, got.az), (want.u, want.w, want.ax, want.az), strict=True):
            close(a, b)
    assert phases.fits(sea.components, offsets) and not phases.fits(sea.components, offsets[:-1])
