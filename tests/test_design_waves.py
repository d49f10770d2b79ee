"""Design waves: NewWave and the constrained NewWave embedded in a random sea (sitl/sea.py), against
independent truth (the spectrum's autocorrelation by quadrature, the requested crest, Table I's Hs)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from bridge.models.waves import WaveComponents, elevation, wavenumber
from sitl.sea import Sea, jonswap_spectrum, load_sea_config

# Published sea states (Walker et al. Table I) as written in configs/sea/*.yaml.
CASES = {"W1": (2.78, 7.1), "W2": (3.47, 9.5), "W3": (3.24, 11.1)}
DEPTH = 54.0



def focused_config(case: str, crest: float, x: float = 0.0, t: float = 120.0) -> dict:
    cfg = load_sea_config(case)
    cfg["focus"] = {"crest": crest, "x": x, "t": t}
    return cfg


@pytest.mark.parametrize("case,crest,x0,seed", [("W1", 4.0, 0.0, 1), ("W2", 4.5, 0.0, 5), ("W2", 6.0, 30.0, 6),
                                                ("W3", 4.0, -10.0, 2)])
def test_focused_sea_has_the_requested_crest_where_and_when_asked(case, crest, x0, seed):
    """ζ(x0, t0), Stokes 2nd-order terms included, is the crest to 1e-9 m, and it is a crest:
    the highest elevation at x0 within ±Tp and over the 600 s record."""
    sea = Sea.from_config(focused_config(case, crest, x0, 120.0), seed)
    assert sea.components.second_order
    assert float(sea.elevation(x0, 120.0)) == pytest.approx(crest, abs=1e-9)
    tp = 2 * np.pi / sea.omega_peak
    t = np.arange(0.0, 600.0, 0.02)
    z = sea.elevation(x0, t)
    near = np.abs(t - 120.0) < tp
    assert z[near].max() <= crest + 1e-9 and z.max() <= crest + 1e-9
    # and, in space, the wave at t0 peaks near x0 (within an eighth of the peak wavelength)
    lam_p = 2 * np.pi / float(wavenumber(np.array([sea.omega_peak]), DEPTH)[0])
    xs = x0 + np.linspace(-lam_p / 2, lam_p / 2, 2001)
    assert abs(xs[np.argmax(sea.elevation(xs, 120.0))] - x0) < lam_p / 8


@pytest.mark.parametrize("case", list(CASES))
def test_newwave_profile_is_the_spectrum_autocorrelation(case):
    """NewWave at the focus: ζ(τ) = α R(τ)/R(0), R(τ) = ∫ S(ω) cos ωτ dω by quadrature of the
    continuous JONSWAP over the discretised band (independent of the discrete components)."""
    from sitl.sea import newwave
    hs, tp = CASES[case]
    cfg = load_sea_config(case)
    sea = Sea.from_config(cfg, 3)
    lin = WaveComponents(sea.components.amplitude, sea.components.omega, sea.components.k,
                         sea.components.phase, DEPTH, False)
    alpha, t0 = 4.0, 50.0
    nw = newwave(lin, alpha, 0.0, t0)
    wp = 2 * np.pi / tp
    lo, hi = np.array(cfg["omega_band"]) * wp

    def R(tau):
        return quad(lambda w: float(jonswap_spectrum(w, hs, tp, cfg["spectrum"]["gamma"])) * np.cos(w * tau),
                    lo, hi, limit=400, points=[wp])[0]
    taus = np.linspace(-2 * tp, 2 * tp, 41)
    truth = alpha * np.array([R(tau) for tau in taus]) / R(0.0)
    got = elevation(nw, 0.0, t0 + taus)
    assert got[20] == pytest.approx(alpha, abs=1e-12)
    assert np.max(np.abs(got - truth)) < 0.015 * alpha
    # a NewWave is symmetric in time about its crest and its troughs are shallower than the crest
    np.testing.assert_allclose(got, got[::-1], atol=1e-9)
    assert -0.75 * alpha < got.min() < 0.0


@pytest.mark.parametrize("case", list(CASES))
def test_focused_sea_keeps_the_spectrum_hs_and_the_newwave_shape(case):
    """Re-phasing keeps every amplitude √(2 S Δω): the realised Hs is the unfocused sea's (within 1 % of
    Table I), the frequencies are unchanged, and near the focus the record follows NewWave."""
    from sitl.sea import newwave
    hs, tp = CASES[case]
    for seed in (1, 5, 6):
        plain = Sea.load(case, seed)
        sea = Sea.from_config(focused_config(case, 4.0), seed)
        assert sea.hs() == pytest.approx(hs, rel=0.01)
        np.testing.assert_array_equal(sea.components.amplitude, plain.components.amplitude)
        np.testing.assert_array_equal(sea.components.omega, plain.components.omega)
        t = 120.0 + np.linspace(-2 * tp, 2 * tp, 401)
        lin = WaveComponents(sea.components.amplitude, sea.components.omega, sea.components.k,
                             sea.components.phase, DEPTH, False)
        corr = np.corrcoef(elevation(lin, 0.0, t), elevation(newwave(lin, 4.0, 0.0, 120.0), 0.0, t))[0, 1]
        assert corr > 0.8, (seed, corr)
        # the record's 4σ over 600 s stays a sea of this Hs, crest or not (sampling within 15 %)
        rec = sea.elevation(0.0, np.arange(0.0, 600.0, 0.25))
        assert 4 * rec.std() == pytest.approx(hs, rel=0.15)


def test_focused_sea_same_seed_same_sea():
    a = Sea.from_config(focused_config("W2", 4.5), 11).components
    b = Sea.from_config(focused_config("W2", 4.5), 11).components
    np.testing.assert_array_equal(a.phase, b.phase)
    assert Sea.from_config(focused_config("W2", 4.5), 11).focus == (4.5, 0.0, 120.0)


@pytest.mark.parametrize("focus,key,allowed", [
    ({"crest": 4.0}, "focus.t", "required"),
    ({"t": 60.0}, "focus.crest", "required"),
    ({"crest": -1.0, "t": 60.0}, "focus.crest", "(0, 30]"),
    ({"crest": 9.0, "t": 60.0}, "focus.crest", "(0, 8.675] m"),
    ({"crest": 4.0, "t": -5.0}, "focus.t", "[0, 100000]"),
    ({"crest": 4.0, "t": 60.0, "phase": 1}, "focus.phase", "unknown key"),
])
def test_focus_config_errors_name_file_key_and_range(tmp_path, focus, key, allowed):
    import yaml

    from bridge.configfile import ConfigError, configs_dir
    data = yaml.safe_load((configs_dir() / "sea" / "W2.yaml").read_text())
    data["focus"] = focus
    path = tmp_path / "focused.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError) as err:
        load_sea_config(path)
    msg = str(err.value)
    assert str(path) in msg and key in msg and allowed in msg
