"""Issue #13's fast paths give what the slow ones gave: to the last bits where the arithmetic is
the same, and within a stated bound where only the order of rounding changed (docs/benchmarks.md)."""
from __future__ import annotations

import numpy as np
import pytest

from bridge import dswp
from sitl.buoy import BuoyTape
from sitl.sea import Sea

_svd_fit = dswp._svd_least_squares   # the former fit: numpy's SVD least squares


def _window_system(case, t_end, oversample, lost):
    """The DSWP fit's columns and record for a 120 s window of the case's buoy ending at t_end."""
    sea = Sea.load(case, seed=2)
    _, eta = sea.buoy().record(t_end - 119.5, t_end)
    if lost:
        eta[np.random.default_rng(7).uniform(size=eta.size) < 0.2] = np.nan
    n, dt = eta.size, 0.5
    tau = (np.arange(n) - (n - 1)) * dt
    filled, present = dswp._fill_gaps(eta)
    omega = dswp._select_frequencies(filled, n, dt, 0.05, 0.5, 0.05, "none", oversample)
    arg = np.multiply.outer(tau, omega)
    cols = np.hstack([np.ones((n, 1)), (tau / (n * dt))[:, None], np.cos(arg), np.sin(arg)])
    if present is not None:
        cols, eta = cols[present], eta[present]
    return cols, eta, omega.size


@pytest.mark.parametrize("case,t_end", [("W1", 0.0), ("W2", 37.5), ("W3", 200.0)])
@pytest.mark.parametrize("oversample,lost", [(1, False), (2, False), (4, False), (1, True), (2, True)])
def test_the_cholesky_fit_gives_the_svd_components(case, t_end, oversample, lost):
    cols, eta, m = _window_system(case, t_end, oversample, lost)
    penalty = 1e-3 * eta.size if oversample > 1 else 0.0
    got, want = dswp._least_squares(cols.copy(), eta, penalty), _svd_fit(cols, eta, penalty)
    amp_got, amp_want = np.hypot(got[2:2 + m], got[2 + m:]), np.hypot(want[2:2 + m], want[2 + m:])
    big = amp_want > 1e-3 * amp_want.max()        # a component's phase is defined by its amplitude
    np.testing.assert_allclose(amp_got, amp_want, rtol=1e-9, atol=1e-12 * amp_want.max())
    np.testing.assert_allclose(np.arctan2(got[2 + m:], got[2:2 + m])[big],
                               np.arctan2(want[2 + m:], want[2:2 + m])[big], rtol=0, atol=1e-9)


def test_an_ill_conditioned_fit_falls_back_to_the_svd():
    cols, eta, _ = _window_system("W1", 0.0, 1, False)
    cols = np.hstack([cols, cols[:, -1:] * (1 + 1e-9)])   # two near-identical columns: κ ≈ 1e18
    np.testing.assert_array_equal(dswp._least_squares(cols.copy(), eta, 0.0), _svd_fit(cols, eta, 0.0))


@pytest.mark.parametrize("overrides", [{}, {"buoy.dropout": 0.2, "buoy.noise_snr_db": 10.0,
                                            "buoy.clock_offset": 0.75}])
def test_the_buoy_tape_records_what_the_buoy_records(overrides):
    sea = Sea.load("W2", seed=3, overrides=overrides)
    buoy = sea.buoy()
    tape = BuoyTape(buoy, block=64)
    for t in np.arange(0.0, 200.0, 0.5):
        t_last = buoy.newest_stamp(t)
        t_want, want = buoy.record(t_last - 120.0, t_last)
        t_got, got = tape.record(t_last - 120.0, t_last)
        np.testing.assert_array_equal(t_got, t_want)
        np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-14)   # rounding of the sum's last bit
    assert len(tape._blocks) <= 120.0 * 2 // 64 + 2                  # old blocks are let go
