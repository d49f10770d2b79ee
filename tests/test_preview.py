"""The saturation preview (firmware_py/control/preview.py): compiled and reference paths agree; it acts only
when the forecast load exceeds the thrusters' authority; it shifts the target ahead of such a group."""
from __future__ import annotations

import numpy as np
import pytest

from bridge.models import kernels
from bridge.models.vehicle import VehicleParams, strip_nodes
from firmware_py.control.preview import N_CANDIDATES, SaturationPreview, preview_excursions
from firmware_py.params.table import load_params
from sitl.harness.results import TIMESERIES_COLUMNS as COLS
from sitl.harness.run import run_mission
from sitl.harness.spec import RunSpec
from sitl.sea import Sea

VEHICLE = VehicleParams.load("bluerov2_heavy")
STRIPS = strip_nodes(VEHICLE.length, 3)


def _excursions(t: float, monkeypatch=None) -> np.ndarray:
    sea = Sea.load("design/W2F")
    cands = np.linspace(-1.0, 1.0, N_CANDIDATES)[:, None] * np.array([0.5, 0.5])
    return preview_excursions(VEHICLE, load_params(), sea.components, np.array([0.0, 5.0, 0.02]),
                              np.array([0.1, -0.2, 0.0]), np.array([0.05, -0.1]), np.array([0.1, 0.2]),
                              cands, t, STRIPS)


@pytest.mark.skipif(not kernels.ENABLED, reason="numba not in use")
def test_compiled_preview_equals_the_reference(monkeypatch):
    compiled = _excursions(55.0)
    monkeypatch.setattr(kernels, "ENABLED", False)
    reference = _excursions(55.0)
    assert compiled.shape == (N_CANDIDATES, 2)
    np.testing.assert_allclose(compiled, reference, rtol=1e-12, atol=1e-12)


def test_preview_predicts_the_focused_crest_and_a_calm_sea():
    """Ahead of the 4.5 m crest the unshifted excursion is metres; 50 s earlier it is centimetres."""
    zero = N_CANDIDATES // 2
    assert _excursions(55.0)[zero, 1] > 1.0
    assert _excursions(5.0)[zero].max() < 0.3


def test_preview_is_off_without_a_forecast_or_when_disabled():
    params = load_params(overrides={"WK_PRV_ENABLE": 0})
    prv = SaturationPreview(VEHICLE, params, STRIPS)
    x_hat = np.array([0.0, 5.0, 0.0, 0.0, 0.0, 0.0])
    sea = Sea.load("design/W2F")
    assert np.all(prv.update(sea.components, x_hat, x_hat[:3], 55.0) == 0.0)
    assert np.all(SaturationPreview(VEHICLE, load_params(), STRIPS).update(None, x_hat, x_hat[:3], 55.0) == 0.0)


def test_preview_never_moves_the_target_in_a_moderate_sea():
    """W1 (Hs 2.8 m): the FF holds the vehicle within the thrusters' authority, so no shift at all."""
    run = run_mission(RunSpec("W1", "cpd_ff", duration=120.0))
    assert run.results["ff_active_fraction"] > 0.95
    for name in ("prv_x", "prv_z"):
        assert np.all(run.timeseries[:, COLS.index(name)] == 0.0), name


def test_preview_shifts_the_target_ahead_of_the_group_and_returns():
    """W2F: the offset moves (slew-limited, within ±WK_PRV_MAX) before the crest at 60 s, is zero at the end."""
    params = load_params()
    ts = run_mission(RunSpec("design/W2F", "cpd_ff", duration=90.0)).timeseries
    t, prv = ts[:, COLS.index("t")], ts[:, [COLS.index("prv_x"), COLS.index("prv_z")]]
    before = (t > 30.0) & (t < 60.0)
    assert np.abs(prv[before]).max() > 0.2
    assert np.all(np.abs(prv) <= [params["WK_PRV_MAX_X"], params["WK_PRV_MAX_Z"]])
    step = np.abs(np.diff(prv, axis=0)).max()
    assert step <= params["WK_PRV_RATE"] * 0.05 + 1e-12                # slew-limited
    assert np.all(prv[t > 85.0] == 0.0)
