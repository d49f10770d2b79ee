"""The reproduce summary: every statement under the table is computed from the rows and names what it covers."""
from __future__ import annotations

import itertools

from sitl.harness.reproduce import format_reproduce_table, summarise

DOFS = ("surge", "heave", "pitch")


def rows(worse: set[tuple[str, str, str]] = frozenset(), cheap: set[tuple[str, str]] = frozenset()) -> list[dict]:
    """Nine results: FF lowers every RMSE by 50 % (15 dB by 20 %) and draws more power, except where told."""
    out = []
    for case, (controller, snr, key) in itertools.product(
            ("W1", "W2", "W3"), (("cpd", None, "cpd"), ("cpd_ff", None, "ff_exact"), ("cpd_ff", 15.0, "ff_snr15"))):
        factor = {"cpd": 1.0, "ff_exact": 0.5, "ff_snr15": 0.8}[key]
        rmse = {d: (1.5 if (case, key, d) in worse else factor) * 0.1 for d in DOFS}
        power = {d: (50.0 if (case, key) in cheap else 100.0 / factor) for d in DOFS}
        label = {"cpd": "C-PD", "ff_exact": "C-PD+FF exact", "ff_snr15": "C-PD+FF 15 dB"}[key]
        out.append({"case": case, "controller": controller, "forecast_snr_db": snr, "label": label,
                    "rmse": rmse, "max_abs_error": dict(rmse), "mean_power_w": power})
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
