"""The reproduce summary: every statement under the table is computed from the rows and names what it covers."""
from __future__ import annotations

import itertools
import math

import pytest

from sitl.harness.reproduce import format_reproduce_table, summarise

DOFS = ("surge", "heave", "pitch")


RMSE_FACTOR = {"cpd": 1.0, "ff_exact": 0.5, "ff_snr15": 0.8}
"""Each variant's RMSE against C-PD's, every case and DoF (FF exact lowers it by 50 %, 15 dB by 20 %)."""
CPD_MAX = {"surge": 0.31, "heave": 0.27, "pitch": 0.09}
"""C-PD's maximum errors (m, m, rad): larger than its RMSE of 0.1, as a maximum is."""
MAX_FACTOR = {"cpd": {c: {d: 1.0 for d in DOFS} for c in ("W1", "W2", "W3")},
              "ff_exact": {c: {"surge": 0.78, "heave": 0.882, "pitch": 0.499} for c in ("W1", "W2", "W3")},
              "ff_snr15": {c: {d: f for d in DOFS} for c, f in (("W1", 0.9), ("W2", 0.95), ("W3", 1.0))}}
"""Each variant's maximum error against C-PD's, per case and DoF: not its RMSE factor, so that a summary
computing one from the other is caught. FF exact's are the paper's per-DoF reductions (22, 11.8, 50.1 %)."""


def rows(worse: set[tuple[str, str, str]] = frozenset(), cheap: set[tuple[str, str]] = frozenset()) -> list[dict]:
    """Nine results: RMSE and maximum error as RMSE_FACTOR and MAX_FACTOR say, and FF draws more power,
    except where told (``worse``: that RMSE is 1.5× C-PD's; ``cheap``: FF draws less power there)."""
    out = []
    for case, (controller, snr, key) in itertools.product(
            ("W1", "W2", "W3"), (("cpd", None, "cpd"), ("cpd_ff", None, "ff_exact"), ("cpd_ff", 15.0, "ff_snr15"))):
        factor = RMSE_FACTOR[key]
        rmse = {d: (1.5 if (case, key, d) in worse else factor) * 0.1 for d in DOFS}
        max_abs_error = {d: MAX_FACTOR[key][case][d] * CPD_MAX[d] for d in DOFS}
        power = {d: (50.0 if (case, key) in cheap else 100.0 / factor) for d in DOFS}
        label = {"cpd": "C-PD", "ff_exact": "C-PD+FF exact", "ff_snr15": "C-PD+FF 15 dB"}[key]
        out.append({"case": case, "controller": controller, "forecast_snr_db": snr, "label": label,
                    "rmse": rmse, "max_abs_error": max_abs_error, "mean_power_w": power})
    return out


def test_the_summary_counts_the_pairs_it_covers():
    res = rows(worse={("W2", "ff_snr15", "pitch")}, cheap={("W3", "ff_exact")})
    s = summarise(res)
    assert s["rmse_lowered"]["ff_exact"] == {"n": 9, "of": 9, "all": True, "where": [f"{c} {d}" for c in
                                             ("W1", "W2", "W3") for d in DOFS], "except": []}
    assert s["rmse_lowered"]["ff_snr15"]["n"] == 8 and s["rmse_lowered"]["ff_snr15"]["except"] == ["W2 pitch"]
    assert s["more_power"]["ff_exact"]["except"] == ["W3"] and not s["ff_draws_more_power"]
    text = format_reproduce_table(res, s)
    assert "FF exact lowers RMSE against C-PD in 9 of 9 (case, DoF) pairs" in text
    assert "FF 15 dB lowers RMSE against C-PD in 8 of 9 (case, DoF) pairs (not in: W2 pitch)" in text
    assert "draws more power than C-PD in 2 of 3 cases (not in: W3)" in text
    assert "all nine" not in text
    assert "means over the 9 (case, DoF) pairs of W1, W2, W3 × surge, heave, pitch" in text


def test_the_reductions_are_each_of_their_own_error():
    """The RMSE reductions come from the RMSEs and the maximum-error reductions (the paper's ≈ 28 %) from the
    maximum errors: per (case, DoF) 100 (1 − factor), and their means over the nine pairs."""
    s = summarise(rows())
    cases = ("W1", "W2", "W3")
    for key in ("ff_exact", "ff_snr15"):
        for c in cases:
            for d in DOFS:
                assert s["rmse_reduction_pct"][key][c][d] == pytest.approx(100.0 * (1.0 - RMSE_FACTOR[key]))
                assert s["max_error_reduction_pct"][key][c][d] == pytest.approx(100.0 * (1.0 - MAX_FACTOR[key][c][d]))
    assert s["mean_rmse_reduction_pct"] == pytest.approx({"ff_exact": 50.0, "ff_snr15": 20.0})
    assert s["mean_max_error_reduction_pct"] == pytest.approx({"ff_exact": (22.0 + 11.8 + 50.1) / 3,
                                                               "ff_snr15": (10.0 + 5.0 + 0.0) / 3})
    text = format_reproduce_table(rows(), s)
    assert "mean RMSE reduction: exact forecast 50.0 % (paper ≈ 48 %), 15 dB forecast 20.0 % (paper ≈ 17 %)" in text
    assert "mean max-error reduction: exact 28.0 % (paper ≈ 28 %), 15 dB 5.0 %" in text
    assert s["worst_excursion"]["W2 C-PD+FF exact"] == pytest.approx(
        {"max_m": 0.78 * 0.31, "max_pitch_deg": math.degrees(0.499 * 0.09)})
